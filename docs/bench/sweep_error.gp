$max_slope_fast << EOD
0.02 0.0459193
0.04 0.246589
0.08 0.787336
0.16 0.621798
0.24 0.953246
0.4 0.425619
EOD
$max_slope_balanced << EOD
0.02 0.0459193
0.04 0.246589
0.08 0.00233363
0.16 0.00172674
0.24 0.0123261
0.4 0.0215377
EOD
$max_slope_accurate << EOD
0.02 0.308935
0.04 0.246589
0.08 0.00233363
0.16 0.00172674
0.24 0.0123261
0.4 0.0215377
EOD
$noise_fast << EOD
200000 0.927452
20000 0.953246
5000 0.911338
2000 0.806587
800 0.846927
300 0.798493
EOD
$noise_balanced << EOD
200000 0.00404809
20000 0.0123261
5000 0.0159333
2000 0.0142106
800 0.846927
300 0.798493
EOD
$noise_accurate << EOD
200000 0.00404809
20000 0.0123261
5000 0.0159333
2000 0.0142106
800 0.840282
300 0.887604
EOD
$blur_fast << EOD
0.3 1.25154
0.6 0.953246
1.2 0.424463
2.4 0.567803
4 1.44166
6 2.76749
EOD
$blur_balanced << EOD
0.3 0.0134745
0.6 0.0123261
1.2 0.00939384
2.4 0.00835838
4 0.0258283
6 0.171771
EOD
$blur_accurate << EOD
0.3 0.0134745
0.6 0.0123261
1.2 0.00939384
2.4 0.00835838
4 0.0258283
6 0.171771
EOD
$px_per_period_fast << EOD
32 4.3548
16 3.18389
8 0.972518
5 0.145733
3 0.131546
2 0.0206048
EOD
$px_per_period_balanced << EOD
32 4.3548
16 0.0103601
8 0.0128184
5 0.00762586
3 0.131546
2 0.0206048
EOD
$px_per_period_accurate << EOD
32 4.3548
16 0.0103601
8 0.0128184
5 0.00762586
3 0.0589874
2 0.0499159
EOD
$phase_angle_fast << EOD
10 0.238923
40 0.174291
70 0.655361
100 0.593138
120 0.707932
EOD
$phase_angle_balanced << EOD
10 0.00130005
40 0.0112326
70 0.00824377
100 0.00867855
120 0.707932
EOD
$phase_angle_accurate << EOD
10 0.00130005
40 0.0112326
70 0.00824377
100 0.00867855
120 0.721568
EOD
$tilt_fast << EOD
0 0.953246
1 0.977471
2 0.887737
3 0.96158
4 0.962089
5 0.942244
EOD
$tilt_balanced << EOD
0 0.0123261
1 0.268852
2 0.266037
3 0.326223
4 0.283494
5 0.942244
EOD
$tilt_accurate << EOD
0 0.0123261
1 0.268852
2 0.266037
3 0.326223
4 0.305289
5 0.919566
EOD
$exposure_fast << EOD
1 0.953246
10 1.40888
EOD
$exposure_balanced << EOD
1 0.0123261
10 0.0175891
30 0.088638
EOD
$exposure_accurate << EOD
1 0.0123261
10 0.0175891
30 0.088638
EOD
set terminal pngcairo size 1900,850 font ',10'
set output '/tmp/w10/sweep/sweep_error.png'
set multiplot layout 2,4 title 'weavefit stability: median |peak spacing error|, deg (a sinusoid, m 0.24, 1.44 mm = 16 px per period, 320x240, alpha 30 deg; one axis varied at a time)'
set grid
set key top left
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'max slope m'
plot $max_slope_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $max_slope_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $max_slope_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'photons at full scale (fewer = noisier)'
plot $noise_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $noise_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $noise_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'source blur sigma, deg'
plot $blur_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $blur_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $blur_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'pixels per thread period'
plot $px_per_period_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $px_per_period_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $px_per_period_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
unset logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'phase angle, deg'
plot $phase_angle_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $phase_angle_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $phase_angle_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
unset logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'axis tilt, deg'
plot $tilt_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $tilt_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $tilt_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'exposure, times the default (glints clip)'
plot $exposure_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $exposure_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $exposure_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
unset multiplot
set terminal svg size 1900,850
set output '/tmp/w10/sweep/sweep_error.svg'
set multiplot layout 2,4 title 'weavefit stability: median |peak spacing error|, deg (a sinusoid, m 0.24, 1.44 mm = 16 px per period, 320x240, alpha 30 deg; one axis varied at a time)'
set grid
set key top left
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'max slope m'
plot $max_slope_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $max_slope_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $max_slope_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'photons at full scale (fewer = noisier)'
plot $noise_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $noise_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $noise_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'source blur sigma, deg'
plot $blur_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $blur_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $blur_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'pixels per thread period'
plot $px_per_period_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $px_per_period_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $px_per_period_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
unset logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'phase angle, deg'
plot $phase_angle_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $phase_angle_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $phase_angle_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
unset logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'axis tilt, deg'
plot $tilt_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $tilt_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $tilt_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'exposure, times the default (glints clip)'
plot $exposure_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $exposure_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $exposure_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
unset multiplot
