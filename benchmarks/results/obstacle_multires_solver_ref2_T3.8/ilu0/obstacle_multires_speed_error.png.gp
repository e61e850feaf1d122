set terminal pngcairo size 900,600 font 'sans,11' noenhanced
set output '/tmp/s72/out_ilu0/obstacle_multires_speed_error.png'
set title 'Dam break with the obstacle, front against 2.00 mm: body_front_rms against wall time (median of runs)'
set xlabel 'wall time (s)'
set ylabel 'body_front_rms'
set logscale xy
set grid
set key top left
set offsets graph 0.05, graph 0.05, graph 0.15, graph 0.15
plot '/tmp/s72/out_ilu0/obstacle_multires_speed_error.png.dat' index 0 using 1:2 with linespoints pt 7 title 'single', '' index 0 using 1:2:3 with labels offset 0,1.2 notitle, \
     '/tmp/s72/out_ilu0/obstacle_multires_speed_error.png.dat' index 1 using 1:2 with linespoints pt 7 title 'multi', '' index 1 using 1:2:3 with labels offset 0,-1.2 notitle
