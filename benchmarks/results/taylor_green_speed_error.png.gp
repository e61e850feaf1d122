set terminal pngcairo size 900,600 font 'sans,11' noenhanced
set output 'benchmarks/results/taylor_green_speed_error.png'
set title 'Taylor-Green vortex: energy_drift against wall time (median of runs)'
set xlabel 'wall time (s)'
set ylabel 'energy_drift'
set logscale xy
set grid
set key top left
set offsets graph 0.05, graph 0.05, graph 0.15, graph 0.15
plot 'benchmarks/results/taylor_green_speed_error.png.dat' index 0 using 1:2 with linespoints pt 7 title 'LSMPS-A order 2', '' index 0 using 1:2:3 with labels offset 0,1.2 notitle
