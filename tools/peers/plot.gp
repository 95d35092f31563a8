# The peer comparison's figures, from pgi_peers' CSV files:
#   gnuplot -e "kind='work-precision'; csv='F.csv'; out='F.svg'; name='rigid body'" tools/peers/plot.gp
#   gnuplot -e "kind='drift'; csv='F.csv'; out='F.svg'; name='rigid body'" tools/peers/plot.gp
# One curve per method found in the CSV (its first column).
set datafile separator ","
set terminal svg size 760,480 font "sans,11" background "white" noenhanced
set key outside right
set grid
set logscale xy
set format x "1e%L"; set format y "1e%L"
set output out
methods = system(sprintf("awk -F, 'NR > 1 && !seen[$1]++ {print $1}' '%s'", csv))
# one colour per method (gnuplot's default cycle repeats after 8); pgi's curves drawn thicker
colors = "#000000 #e41a1c #377eb8 #4daf4a #984ea3 #ff7f00 #a65628 #f781bf #17becf #999999 #bcbd22 #1b9e77"
color(i) = word(colors, (i - 1) % words(colors) + 1)
width(m) = strstrt(m, "pgi") == 1 ? 3 : 1.5

if (kind eq "work-precision") {
    set title "work-precision, ".name." (T = 100)"
    set xlabel "wall time (s, best of 3)"; set ylabel "final error (max norm)"
    plot for [i=1:words(methods)] sprintf("< awk -F, '$1==\"%s\" && $9==1' '%s'", word(methods,i), csv) using 4:3 \
         with linespoints lc rgb color(i) lw width(word(methods,i)) pt i title word(methods,i)
} else {
    set title "long run, ".name.": relative errors of the invariants against t"
    set xlabel "t (log scale)"; set ylabel "relative error (log scale)"
    # the line styles explained in the key, then one colour per method; the dotted grey line is the unit
    # round-off u = 2^-53, below which no relative error of a double can be resolved
    plot NaN with lines lc rgb "black" lw 1.5 title "relative error of H (solid)", \
         NaN with lines lc rgb "black" lw 1.5 dt 2 title "of the Casimir (dashed)", \
         2.0**-53 with lines lc rgb "#777777" dt 3 lw 1.5 title "unit round-off u = 2^-53", \
         for [i=1:words(methods)] sprintf("< awk -F, '$1==\"%s\" && $3>0' '%s'", word(methods,i), csv) using 2:3 with lines lc rgb color(i) lw width(word(methods,i)) title word(methods,i), \
         for [i=1:words(methods)] sprintf("< awk -F, '$1==\"%s\" && $4>0' '%s'", word(methods,i), csv) using 2:4 with lines lc rgb color(i) lw width(word(methods,i)) dt 2 notitle
}
