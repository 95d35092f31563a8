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

if (kind eq "work-precision") {
    set title "work-precision, ".name." (T = 100)"
    set xlabel "wall time (s, best of 3)"; set ylabel "final error (max norm)"
    plot for [m in methods] sprintf("< awk -F, '$1==\"%s\" && $9==1' '%s'", m, csv) using 4:3 with linespoints title m
} else {
    set title "long run, ".name.": relative energy error (solid), Casimir error (dashed)"
    set xlabel "t"; set ylabel "relative error"
    plot for [i=1:words(methods)] sprintf("< awk -F, '$1==\"%s\" && $3>0' '%s'", word(methods,i), csv) using 2:3 with lines lc i lw 2 title word(methods,i), \
         for [i=1:words(methods)] sprintf("< awk -F, '$1==\"%s\" && $4>0' '%s'", word(methods,i), csv) using 2:4 with lines lc i dt 2 notitle
}
