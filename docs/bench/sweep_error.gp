$max_slope_fast << EOD
0.02 0.049238
0.04 0.25086
0.08 0.784902
0.16 0.626675
0.24 0.944938
0.4 0.437245
EOD
$max_slope_balanced << EOD
0.02 0.049238
0.04 0.25086
0.08 0.0130187
0.16 0.019679
0.24 0.0461933
0.4 0.0722941
EOD
$max_slope_accurate << EOD
0.02 0.309703
0.04 0.25086
0.08 0.0130187
0.16 0.019679
0.24 0.0461933
0.4 0.0722941
EOD
$noise_fast << EOD
200000 0.923887
20000 0.944938
5000 0.896865
2000 0.785364
800 0.862675
300 1.24738
EOD
$noise_balanced << EOD
200000 0.0322751
20000 0.0461933
5000 0.0614968
2000 0.106345
800 0.862675
300 1.24738
EOD
$noise_accurate << EOD
200000 0.0322751
20000 0.0461933
5000 0.0614968
2000 0.106345
800 0.811464
300 1.00306
EOD
$blur_fast << EOD
0.3 1.24002
0.6 0.944938
1.2 0.413254
2.4 0.56419
4 1.43765
6 2.7613
EOD
$blur_balanced << EOD
0.3 0.0828621
0.6 0.0461933
1.2 0.0413705
2.4 0.0204922
4 0.0835362
6 0.156557
EOD
$blur_accurate << EOD
0.3 0.0828621
0.6 0.0461933
1.2 0.0413705
2.4 0.0204922
4 0.0835362
6 0.156557
EOD
$px_per_period_fast << EOD
32 4.95279
16 3.17181
8 0.963619
5 0.157289
3 0.119494
2 0.0293356
EOD
$px_per_period_balanced << EOD
32 4.95279
16 0.0232719
8 0.0439907
5 0.0705131
3 0.119494
2 0.0293356
EOD
$px_per_period_accurate << EOD
32 4.95279
16 0.0232719
8 0.0439907
5 0.0705131
3 0.049772
2 0.0407588
EOD
$phase_angle_fast << EOD
10 0.130493
40 0.242095
70 0.648951
100 0.620516
120 0.569474
EOD
$phase_angle_balanced << EOD
10 0.0355791
40 0.0447032
70 0.0557522
100 0.115528
120 0.569474
EOD
$phase_angle_accurate << EOD
10 0.0355791
40 0.0447032
70 0.0557522
100 0.101667
120 0.596782
EOD
$tilt_fast << EOD
0 0.944938
1 0.970646
2 0.885326
3 0.95689
4 0.953055
5 0.938365
EOD
$tilt_balanced << EOD
0 0.0461933
1 0.319186
2 0.20853
3 0.286494
4 0.293747
5 0.938365
EOD
$tilt_accurate << EOD
0 0.0461933
1 0.319186
2 0.20853
3 0.286494
4 0.322224
5 0.92037
EOD
$exposure_fast << EOD
1 0.944938
10 3.49454
EOD
$exposure_balanced << EOD
1 0.0461933
10 0.0450269
100 0.0547613
EOD
$exposure_accurate << EOD
1 0.0461933
10 0.0450269
100 0.0547613
EOD
set terminal pngcairo size 1900,850 font ',10'
set output '/tmp/sweep_E/sweep_error.png'
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
set output '/tmp/sweep_E/sweep_error.svg'
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
