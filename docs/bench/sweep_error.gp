$max_slope_fast << EOD
0.02 0.0474081
0.04 0.252058
0.08 0.787047
0.16 0.622778
0.24 0.952729
0.4 0.427057
EOD
$max_slope_balanced << EOD
0.02 0.0474081
0.04 0.252058
0.08 0.010359
0.16 0.0144731
0.24 0.0342989
0.4 0.0632855
EOD
$max_slope_accurate << EOD
0.02 0.308192
0.04 0.252058
0.08 0.010359
0.16 0.0144731
0.24 0.0342989
0.4 0.0632855
EOD
$noise_fast << EOD
200000 0.926883
20000 0.952729
5000 0.907664
2000 0.794043
800 0.860182
300 1.30156
EOD
$noise_balanced << EOD
200000 0.0296192
20000 0.0342989
5000 0.0458982
2000 0.0456635
800 0.860182
300 1.30156
EOD
$noise_accurate << EOD
200000 0.0296192
20000 0.0342989
5000 0.0458982
2000 0.0456635
800 0.830527
300 1.10748
EOD
$blur_fast << EOD
0.3 1.24943
0.6 0.952729
1.2 0.423323
2.4 0.5673
4 1.43693
6 2.7661
EOD
$blur_balanced << EOD
0.3 0.0255035
0.6 0.0342989
1.2 0.0270597
2.4 0.0312137
4 0.0668778
6 0.196932
EOD
$blur_accurate << EOD
0.3 0.0255035
0.6 0.0342989
1.2 0.0270597
2.4 0.0312137
4 0.0668778
6 0.196932
EOD
$px_per_period_fast << EOD
32 4.35466
16 3.18281
8 0.971156
5 0.148942
3 0.128668
2 0.0206026
EOD
$px_per_period_balanced << EOD
32 4.35466
16 0.0187679
8 0.0346649
5 0.0708449
3 0.128668
2 0.0206026
EOD
$px_per_period_accurate << EOD
32 4.35466
16 0.0187679
8 0.0346649
5 0.0708449
3 0.0553088
2 0.0481061
EOD
$phase_angle_fast << EOD
10 0.135065
40 0.249818
70 0.652753
100 0.597162
120 0.707769
EOD
$phase_angle_balanced << EOD
10 0.0297362
40 0.036853
70 0.0476614
100 0.0707018
120 0.707769
EOD
$phase_angle_accurate << EOD
10 0.0297362
40 0.036853
70 0.0476614
100 0.0707018
120 0.72957
EOD
$tilt_fast << EOD
0 0.952729
1 0.979584
2 0.887047
3 0.960018
4 0.961613
5 0.941725
EOD
$tilt_balanced << EOD
0 0.0342989
1 0.265196
2 0.253812
3 0.299881
4 0.284254
5 0.941725
EOD
$tilt_accurate << EOD
0 0.0342989
1 0.265196
2 0.253812
3 0.299881
4 0.307587
5 0.927529
EOD
$exposure_fast << EOD
1 0.952729
10 1.38869
EOD
$exposure_balanced << EOD
1 0.0342989
10 0.036609
30 0.046824
300 0.228031
EOD
$exposure_accurate << EOD
1 0.0342989
10 0.036609
30 0.046824
300 0.228031
EOD
set terminal pngcairo size 1900,850 font ',10'
set output '/tmp/w2/sweep/sweep_error.png'
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
set output '/tmp/w2/sweep/sweep_error.svg'
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
