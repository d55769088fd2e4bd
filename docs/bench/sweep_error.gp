$max_slope_fast << EOD
0.02 0.046258
0.04 0.246592
0.08 0.787331
0.16 0.621846
0.24 0.953246
0.4 0.425731
EOD
$max_slope_balanced << EOD
0.02 0.046258
0.04 0.246592
0.08 0.00237162
0.16 0.0013882
0.24 0.0122837
0.4 0.0234188
EOD
$max_slope_accurate << EOD
0.02 0.307075
0.04 0.246592
0.08 0.00237162
0.16 0.0013882
0.24 0.0122837
0.4 0.0234188
EOD
$noise_fast << EOD
200000 0.927427
20000 0.953246
5000 0.911439
2000 0.806691
800 0.869688
300 1.31005
EOD
$noise_balanced << EOD
200000 0.00416571
20000 0.0122837
5000 0.0158824
2000 0.0181453
800 0.869688
300 1.31005
EOD
$noise_accurate << EOD
200000 0.00416571
20000 0.0122837
5000 0.0158824
2000 0.0181453
800 0.842762
300 1.1245
EOD
$blur_fast << EOD
0.3 1.25143
0.6 0.953246
1.2 0.424539
2.4 0.568545
4 1.4414
6 2.76655
EOD
$blur_balanced << EOD
0.3 0.0234397
0.6 0.0122837
1.2 0.0086437
2.4 0.0137631
4 0.0531811
6 0.171839
EOD
$blur_accurate << EOD
0.3 0.0234397
0.6 0.0122837
1.2 0.0086437
2.4 0.0137631
4 0.0531811
6 0.171839
EOD
$px_per_period_fast << EOD
32 4.35483
16 3.18397
8 0.972567
5 0.145709
3 0.131502
2 0.0205562
EOD
$px_per_period_balanced << EOD
32 4.35483
16 0.0116262
8 0.0127372
5 0.00272198
3 0.131502
2 0.0205562
EOD
$px_per_period_accurate << EOD
32 4.35483
16 0.0116262
8 0.0127372
5 0.00272198
3 0.0561219
2 0.0512771
EOD
$phase_angle_fast << EOD
10 0.144903
40 0.250241
70 0.655008
100 0.593201
120 0.707769
EOD
$phase_angle_balanced << EOD
10 0.00561392
40 0.0110666
70 0.0100193
100 0.00248267
120 0.375173
EOD
$phase_angle_accurate << EOD
10 0.00561392
40 0.0110666
70 0.0100193
100 0.00248267
120 0.352797
EOD
$tilt_fast << EOD
0 0.953246
1 0.977836
2 0.88769
3 0.961575
4 0.962106
5 0.946767
EOD
$tilt_balanced << EOD
0 0.0122837
1 0.265156
2 0.277474
3 0.326277
4 0.284701
5 0.946767
EOD
$tilt_accurate << EOD
0 0.0122837
1 0.265156
2 0.277474
3 0.326277
4 0.308019
5 0.927529
EOD
$exposure_fast << EOD
1 0.953246
10 1.40886
EOD
$exposure_balanced << EOD
1 0.0122837
10 0.017464
30 0.0436394
300 0.147785
EOD
$exposure_accurate << EOD
1 0.0122837
10 0.017464
30 0.0436394
300 0.147785
EOD
set terminal pngcairo size 1900,850 font ',10'
set output '/tmp/w3/sweep/sweep_error.png'
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
set output '/tmp/w3/sweep/sweep_error.svg'
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
