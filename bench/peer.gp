# bench/peer.gp — manyrods against PyElastica at equal error, from peer.csv
# (manyrods-accuracy --peer DIR writes manyrods' rows; the other code's
# driver appends its own; bench/RESULTS.md "Speed at equal error").
#   gnuplot -e "dir='bench/results/<machine>'" bench/peer.gp   → dir/peer.png
if (!exists("dir")) dir = "."
set datafile separator ","
set terminal pngcairo size 1400,600 noenhanced font ",10"
set output dir."/peer.png"
set multiplot layout 1,2
set logscale xy
set grid
set key top right font ",9"
set format y "%.0e"
# columns: code,case,precision,dt,elements,wall_s,sim_s_per_wall_s,error
sel(code, c, p) = (strcol(1) eq code && strcol(2) eq c && strcol(3) eq p) ? $8 : NaN
set title "struck seed cantilever, undamped, 2 s: max tip error / L against wall time (one rod, one core)"
set xlabel "wall time for 2 simulated seconds, s"
set ylabel "max tip error / L over 2 s"
plot \
  dir."/peer.csv" using 6:(sel("manyrods","struck","double")):5 skip 1 with points pt 7 title "manyrods, double (label: elements)", \
  dir."/peer.csv" using 6:(sel("manyrods","struck","float")) skip 1 with points pt 6 title "manyrods, float", \
  dir."/peer.csv" using 6:(sel("pyelastica","struck","double")) skip 1 with linespoints pt 5 title "PyElastica, float64", \
  dir."/peer.csv" using 6:(sel("manyrods","struck","double")):5 skip 1 with labels offset 0,1 notitle, \
  dir."/peer.csv" using 6:(sel("pyelastica","struck","double")):5 skip 1 with labels offset 0,-1 notitle
set title "hair strand (n = 32) swinging under gravity: tip error / L against simulated s per wall s"
set xlabel "simulated seconds per wall second (one rod, one core)"
set ylabel "max tip error / L (manyrods over 1 s; PyElastica over its run)"
set key bottom right
plot \
  dir."/peer.csv" using 7:(sel("manyrods","hair","double")) skip 1 with points pt 7 title "manyrods stiff rods, double", \
  dir."/peer.csv" using 7:(sel("manyrods","hair","float")) skip 1 with points pt 6 title "manyrods stiff rods, float", \
  dir."/peer.csv" using 7:(sel("manyrods","hair-explicit","double")) skip 1 with points pt 9 ps 2 title "manyrods plain explicit, double", \
  dir."/peer.csv" using 7:(sel("pyelastica","hair","double")) skip 1 with points pt 5 ps 2 title "PyElastica, float64"
unset multiplot
