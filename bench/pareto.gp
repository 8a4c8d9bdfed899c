# bench/pareto.gp — error against cost from manyrods-accuracy's pareto.csv.
#   gnuplot -e "dir='bench/results/<machine>'" bench/pareto.gp   → dir/pareto.png
if (!exists("dir")) dir = "."
set datafile separator ","
set terminal pngcairo size 1400,600 noenhanced font ",10"
set output dir."/pareto.png"
set multiplot layout 1,2
set logscale xy
set grid
set xlabel "wall time, s (one rod, one thread)"
set ylabel "max tip error / L over 1 s"
set key bottom left font ",8"
set format y "%.0e"
# columns: case,integrator,precision,dt,elements,options,wall_s,element_steps_per_s,error
sel(c, i, p, o) = (strcol(1) eq c && strcol(2) eq i && strcol(3) eq p && strcol(6) eq o) ? $9 : NaN
set title "seed cantilever released from 0.05 N, tau = 0.02 s (reference: n = 160/320 Richardson)"
plot \
  dir."/pareto.csv" using 7:(sel("cantilever","position_verlet","double","kv=implicit")) skip 1 with points pt 7 title "Verlet, double, KV implicit", \
  dir."/pareto.csv" using 7:(sel("cantilever","position_verlet","float","kv=implicit")) skip 1 with points pt 6 title "Verlet, float, KV implicit", \
  dir."/pareto.csv" using 7:(sel("cantilever","pefrl","double","kv=implicit")) skip 1 with points pt 5 title "PEFRL, double, KV implicit", \
  dir."/pareto.csv" using 7:(sel("cantilever","pefrl","float","kv=implicit")) skip 1 with points pt 4 title "PEFRL, float, KV implicit", \
  dir."/pareto.csv" using 7:(sel("cantilever","position_verlet","double","kv=explicit")) skip 1 with points pt 9 title "Verlet, double, KV explicit", \
  dir."/pareto.csv" using 7:(sel("cantilever","position_verlet","float","kv=explicit")) skip 1 with points pt 8 title "Verlet, float, KV explicit", \
  dir."/pareto.csv" using 7:(sel("cantilever","position_verlet","double","kv=off")) skip 1 with points pt 3 title "Verlet, double, KV off"
set title "hair n = 32 swinging under gravity (reference: explicit at 2e-8 s)"
plot \
  dir."/pareto.csv" using 7:(sel("hair","position_verlet","double","stiff=implicit")) skip 1 with linespoints pt 7 title "stiff rods, double", \
  dir."/pareto.csv" using 7:(sel("hair","position_verlet","float","stiff=implicit")) skip 1 with linespoints pt 6 title "stiff rods, float", \
  dir."/pareto.csv" using 7:(sel("hair","position_verlet","double","stiff=off (explicit)")) skip 1 with points pt 5 ps 2 title "plain explicit, double", \
  dir."/pareto.csv" using 7:(sel("hair","position_verlet","float","stiff=off (explicit)")) skip 1 with points pt 4 ps 2 title "plain explicit, float"
unset multiplot
