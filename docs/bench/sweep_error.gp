$max_slope_fast << EOD
0.02 0.049238
0.04 0.25086
0.08 0.784902
0.16 0.652135
0.24 0.792031
0.4 0.417932
EOD
$max_slope_balanced << EOD
0.02 0.049238
0.04 0.25086
0.08 0.0130187
0.16 0.0189753
0.24 0.0481265
0.4 0.0695191
EOD
$max_slope_accurate << EOD
0.02 0.309703
0.04 0.25086
0.08 0.0130187
0.16 0.0189753
0.24 0.0481265
0.4 0.0695191
EOD
$noise_fast << EOD
200000 0.869131
20000 0.792031
5000 0.821278
2000 0.725073
800 0.810028
300 1.24738
EOD
$noise_balanced << EOD
200000 0.03323
20000 0.0481265
5000 0.0624586
2000 0.106345
800 0.810028
300 1.24738
EOD
$noise_accurate << EOD
200000 0.03323
20000 0.0481265
5000 0.0624586
2000 0.106345
800 0.811488
300 1.00306
EOD
$blur_fast << EOD
0.3 1.09692
0.6 0.792031
1.2 0.527676
2.4 0.578726
4 1.28122
6 2.60744
EOD
$blur_balanced << EOD
0.3 0.0315998
0.6 0.0481265
1.2 0.0384115
2.4 0.0204937
4 0.0836357
6 0.0766785
EOD
$blur_accurate << EOD
0.3 0.0315998
0.6 0.0481265
1.2 0.0384115
2.4 0.0204937
4 0.0836357
6 0.0766785
EOD
$px_per_period_fast << EOD
32 4.75264
16 3.00731
8 0.966515
5 0.178861
3 0.163822
2 0.0293356
EOD
$px_per_period_balanced << EOD
32 4.75264
16 0.0240479
8 0.0498594
5 0.071463
3 0.163822
2 0.0293356
EOD
$px_per_period_accurate << EOD
32 4.75264
16 0.0240479
8 0.0498594
5 0.071463
3 0.0497741
2 0.0407588
EOD
$phase_angle_fast << EOD
10 0.229686
40 0.355488
70 0.607818
100 0.563405
120 0.580315
EOD
$phase_angle_balanced << EOD
10 0.038648
40 0.0510533
70 0.0557242
100 0.107988
120 0.580315
EOD
$phase_angle_accurate << EOD
10 0.038648
40 0.0510533
70 0.0557242
100 0.107988
120 0.596783
EOD
$tilt_fast << EOD
0 0.792031
1 0.80487
2 0.736403
3 0.86901
4 0.788036
5 0.827494
EOD
$tilt_balanced << EOD
0 0.0481265
1 0.0200365
2 0.39435
3 0.213189
4 0.385077
5 0.375938
EOD
$tilt_accurate << EOD
0 0.0481265
1 0.0200365
2 0.253313
3 0.213189
4 0.321728
5 0.200536
EOD
set terminal pngcairo size 1500,850 font ',10'
set output 'docs/bench/sweep_error.png'
set multiplot layout 2,3 title 'weavefit stability: median |peak spacing error|, deg (a sinusoid, m 0.24, 1.44 mm = 16 px per period, 320x240, alpha 30 deg; one axis varied at a time)'
set grid
set key top left
set logscale x
set logscale y
set yrange [0.005:30]
set xlabel 'max slope m'
plot $max_slope_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $max_slope_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $max_slope_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
set logscale x
set logscale y
set yrange [0.005:30]
set xlabel 'photons at full scale (fewer = noisier)'
plot $noise_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $noise_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $noise_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
set logscale x
set logscale y
set yrange [0.005:30]
set xlabel 'source blur sigma, deg'
plot $blur_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $blur_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $blur_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
set logscale x
set logscale y
set yrange [0.005:30]
set xlabel 'pixels per thread period'
plot $px_per_period_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $px_per_period_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $px_per_period_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
unset logscale x
set logscale y
set yrange [0.005:30]
set xlabel 'phase angle, deg'
plot $phase_angle_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $phase_angle_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $phase_angle_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
unset logscale x
set logscale y
set yrange [0.005:30]
set xlabel 'axis tilt, deg'
plot $tilt_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $tilt_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $tilt_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
unset multiplot
set terminal svg size 1500,850
set output 'docs/bench/sweep_error.svg'
set multiplot layout 2,3 title 'weavefit stability: median |peak spacing error|, deg (a sinusoid, m 0.24, 1.44 mm = 16 px per period, 320x240, alpha 30 deg; one axis varied at a time)'
set grid
set key top left
set logscale x
set logscale y
set yrange [0.005:30]
set xlabel 'max slope m'
plot $max_slope_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $max_slope_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $max_slope_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
set logscale x
set logscale y
set yrange [0.005:30]
set xlabel 'photons at full scale (fewer = noisier)'
plot $noise_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $noise_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $noise_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
set logscale x
set logscale y
set yrange [0.005:30]
set xlabel 'source blur sigma, deg'
plot $blur_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $blur_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $blur_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
set logscale x
set logscale y
set yrange [0.005:30]
set xlabel 'pixels per thread period'
plot $px_per_period_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $px_per_period_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $px_per_period_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
unset logscale x
set logscale y
set yrange [0.005:30]
set xlabel 'phase angle, deg'
plot $phase_angle_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $phase_angle_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $phase_angle_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
unset logscale x
set logscale y
set yrange [0.005:30]
set xlabel 'axis tilt, deg'
plot $tilt_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $tilt_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $tilt_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
unset multiplot
