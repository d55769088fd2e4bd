$max_slope_fast << EOD
0.02 0.0480126
0.04 0.253207
0.08 0.781581
0.16 0.625224
0.24 0.950116
0.4 0.42769
EOD
$max_slope_balanced << EOD
0.02 0.0480126
0.04 0.253207
0.08 0.010962
0.16 0.0520138
0.24 0.0357583
0.4 0.121838
EOD
$max_slope_accurate << EOD
0.02 0.308157
0.04 0.253207
0.08 0.010962
0.16 0.0520138
0.24 0.0357583
0.4 0.121838
EOD
$noise_fast << EOD
200000 0.926536
20000 0.950116
5000 0.90499
2000 0.782533
800 0.855072
300 1.29669
EOD
$noise_balanced << EOD
200000 0.0316759
20000 0.0357583
5000 0.0572744
2000 0.0659365
800 0.855072
300 1.29669
EOD
$noise_accurate << EOD
200000 0.0316759
20000 0.0357583
5000 0.0572744
2000 0.0659365
800 0.817096
300 1.09609
EOD
$blur_fast << EOD
0.3 1.24637
0.6 0.950116
1.2 0.41866
2.4 0.566677
4 1.43477
6 2.76533
EOD
$blur_balanced << EOD
0.3 0.0277547
0.6 0.0357583
1.2 0.0260227
2.4 0.0333123
4 0.0796324
6 0.09249
EOD
$blur_accurate << EOD
0.3 0.0277547
0.6 0.0357583
1.2 0.0260227
2.4 0.0333123
4 0.0796324
6 0.09249
EOD
$px_per_period_fast << EOD
32 4.35431
16 3.18132
8 0.923279
5 0.14788
3 0.126859
2 0.0208769
EOD
$px_per_period_balanced << EOD
32 4.35431
16 0.0359049
8 0.037086
5 0.0610736
3 0.126859
2 0.0208769
EOD
$px_per_period_accurate << EOD
32 4.35431
16 0.0359049
8 0.037086
5 0.0610736
3 0.0544125
2 0.0467851
EOD
$phase_angle_fast << EOD
10 0.319999
40 0.248201
70 0.651417
100 0.599433
120 0.70767
EOD
$phase_angle_balanced << EOD
10 0.0299175
40 0.0390695
70 0.0508102
100 0.0839463
120 0.70767
EOD
$phase_angle_accurate << EOD
10 0.0299175
40 0.0390695
70 0.0508102
100 0.0839463
120 0.729468
EOD
$tilt_fast << EOD
0 0.950116
1 0.978576
2 0.882507
3 0.957916
4 0.959858
5 0.940248
EOD
$tilt_balanced << EOD
0 0.0357583
1 0.262578
2 0.254353
3 0.286634
4 0.28271
5 0.940248
EOD
$tilt_accurate << EOD
0 0.0357583
1 0.262578
2 0.254353
3 0.286634
4 0.305866
5 0.925875
EOD
$exposure_fast << EOD
1 0.950116
10 1.42643
EOD
$exposure_balanced << EOD
1 0.0357583
10 0.0440278
30 0.141407
300 0.185528
EOD
$exposure_accurate << EOD
1 0.0357583
10 0.0440278
30 0.141407
300 0.185528
EOD
set terminal pngcairo size 1900,850 font ',10'
set output '/tmp/w/sweep9/sweep_error.png'
set multiplot layout 2,4 title 'weavefit stability: median |peak spacing error|, deg (a sinusoid, m 0.24, 1.44 mm = 16 px per period, 320x240, alpha 30 deg; one axis varied at a time)'
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
set logscale x
set logscale y
set yrange [0.005:30]
set xlabel 'exposure, times the default (glints clip)'
plot $exposure_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $exposure_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $exposure_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
unset multiplot
set terminal svg size 1900,850
set output '/tmp/w/sweep9/sweep_error.svg'
set multiplot layout 2,4 title 'weavefit stability: median |peak spacing error|, deg (a sinusoid, m 0.24, 1.44 mm = 16 px per period, 320x240, alpha 30 deg; one axis varied at a time)'
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
set logscale x
set logscale y
set yrange [0.005:30]
set xlabel 'exposure, times the default (glints clip)'
plot $exposure_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $exposure_balanced using 1:2 with linespoints lw 2 pt 7 title 'comb fit or peaks (balanced)', $exposure_accurate using 1:2 with linespoints lw 2 pt 9 title 'least squares + comb (accurate)'
unset multiplot
