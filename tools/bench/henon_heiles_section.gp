# The Henon-Heiles Poincare section written by pgi_section_henon_heiles:
# gnuplot -e "csv='...'; out='docs/figures/henon_heiles-section.png'; energy='1/8'" tools/bench/henon_heiles_section.gp
set terminal pngcairo size 800,800 font "sans,11"
set output out
set datafile separator ","
set title sprintf("Henon-Heiles, E = %s: section q1 = 0, p1 > 0 (200 orbits, pgi k = 4, dt = 0.1)", energy)
set xlabel "q2"
set ylabel "p2"
set size ratio -1
set key off
plot csv every ::1 using 3:4 with points pt 7 ps 0.12 lc rgb "#1f4e99"
