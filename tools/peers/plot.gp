# gnuplot -e "scene='rigid_body'; dir='docs/figures'" tools/peers/plot.gp
set datafile separator ","
set terminal svg size 720,480 font "sans,11" background "white" noenhanced
set key outside right
set grid

set output dir."/".scene."-work-precision.svg"
set title "work-precision, ".scene." (T = 100)"
set logscale xy
set format x "1e%L"; set format y "1e%L"
set xlabel "wall time (s)"; set ylabel "final error (max norm)"
methods = "pgi-k2 pgi-k4 pgi-k6 rk2imp rk4imp rk8pd rkf45 msbdf odeint-rk4 odeint-dopri5 odeint-bs"
file = dir."/".scene."-work-precision.csv"
plot for [m in methods] sprintf("< awk -F, '$1==\"%s\" && $9==1' %s", m, file) using 4:3 with linespoints title m

set output dir."/".scene."-drift.svg"
set title "long run, ".scene.": relative energy error (solid) and Casimir error (dashed)"
set xlabel "t"; set ylabel "relative error"
drifts = "pgi-k4 rk4imp rk8pd-1e-12 msbdf-1e-12 odeint-dopri5-1e-12 odeint-bs-1e-12"
file = dir."/".scene."-drift.csv"
plot for [i=1:words(drifts)] sprintf("< awk -F, '$1==\"%s\" && $3>0' %s", word(drifts,i), file) using 2:3 with lines lc i lw 2 title word(drifts,i), \
     for [i=1:words(drifts)] sprintf("< awk -F, '$1==\"%s\" && $4>0' %s", word(drifts,i), file) using 2:4 with lines lc i dt 2 notitle
