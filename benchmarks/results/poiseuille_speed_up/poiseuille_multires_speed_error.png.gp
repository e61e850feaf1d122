set terminal pngcairo size 900,600 font 'sans,11' noenhanced
set output 'benchmarks/results/poiseuille_speed_up/poiseuille_multires_speed_error.png'
set title 'Poiseuille: series against wall time (median of runs)'
set xlabel 'wall time (s)'
set ylabel 'series'
set logscale xy
set grid
set key top left
set offsets graph 0.05, graph 0.05, graph 0.15, graph 0.15
plot 'benchmarks/results/poiseuille_speed_up/poiseuille_multires_speed_error.png.dat' index 0 using 1:2 with linespoints pt 7 title 'periodic body force', '' index 0 using 1:2:3 with labels offset 0,1.2 notitle, \
     'benchmarks/results/poiseuille_speed_up/poiseuille_multires_speed_error.png.dat' index 1 using 1:2 with linespoints pt 7 title 'pressure boundaries 20 mm', '' index 1 using 1:2:3 with labels offset 0,-1.2 notitle, \
     'benchmarks/results/poiseuille_speed_up/poiseuille_multires_speed_error.png.dat' index 2 using 1:2 with linespoints pt 7 title 'periodic body force 2:1', '' index 2 using 1:2:3 with labels offset 0,1.2 notitle, \
     'benchmarks/results/poiseuille_speed_up/poiseuille_multires_speed_error.png.dat' index 3 using 1:2 with linespoints pt 7 title 'pressure boundaries 20 mm 2:1', '' index 3 using 1:2:3 with labels offset 0,-1.2 notitle
