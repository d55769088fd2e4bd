set datafile separator ','
set key off
set logscale xy
set xlabel 'median time per photograph, ms (in-process, decode included; bars: quartiles)'
set ylabel 'median |peak spacing error|, deg (bars: quartiles)'
set title 'weavefit: speed against accuracy over 40 photographs'
set grid
set offsets graph 0.1, graph 0.6, graph 0.3, graph 0.3
plot_it = "plot 'docs/bench/summary.csv' every ::1 using 6:9:7:8:10:11 with xyerrorbars pt 7 ps 1.5 lw 2, 'docs/bench/summary.csv' every ::1 using 6:($9*(int($0)%2 == 0 ? 1.7 : 0.55)):2 with labels left offset 1.5,0 font ',10'"
set terminal pngcairo size 900,600
set output 'docs/bench/speed_accuracy.png'
eval plot_it
set terminal svg size 900,600
set output 'docs/bench/speed_accuracy.svg'
eval plot_it
