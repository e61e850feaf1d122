set terminal pngcairo size 900,600 font 'sans,11' noenhanced
set output 'benchmarks/results/dam_break_tpocml_T3.2/dam_break_speed_error.png'
set title 'Dam break (Koshizuka & Oka; LSMPS in Tanaka''s vessel): front_rms against wall time (median of runs)'
set xlabel 'wall time (s)'
set ylabel 'front_rms'
set logscale x
set grid
set key top left
set offsets graph 0.05, graph 0.05, graph 0.15, graph 0.15
plot 'benchmarks/results/dam_break_tpocml_T3.2/dam_break_speed_error.png.dat' index 0 using 1:2 with linespoints pt 7 title 'cg_ichol', '' index 0 using 1:2:3 with labels offset 0,1.2 notitle, \
     'benchmarks/results/dam_break_tpocml_T3.2/dam_break_speed_error.png.dat' index 1 using 1:2 with linespoints pt 7 title 'LSMPS-A order 2, two-point rows + wall-only shifting + active set with copies + own-loop guard, cond1(M) <= 1e4, shifted velocity limited (Tanaka''s vessel)', '' index 1 using 1:2:3 with labels offset 0,-1.2 notitle
