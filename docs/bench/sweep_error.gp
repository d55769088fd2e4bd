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
0.08 0.00248449
0.16 0.00137563
0.24 0.00769408
0.4 0.0247488
EOD
$max_slope_accurate << EOD
0.02 0.308192
0.04 0.252058
0.08 0.00248449
0.16 0.00137563
0.24 0.00769408
0.4 0.0247488
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
200000 0.00362502
20000 0.00769408
5000 0.0201976
2000 0.0226954
800 0.860182
300 1.30156
EOD
$noise_accurate << EOD
200000 0.00362502
20000 0.00769408
5000 0.0201976
2000 0.0226954
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
0.3 0.0266923
0.6 0.00769408
1.2 0.00634727
2.4 0.013367
4 0.0540954
6 0.171839
EOD
$blur_accurate << EOD
0.3 0.0266923
0.6 0.00769408
1.2 0.00634727
2.4 0.013367
4 0.0540954
6 0.171839
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
16 0.0124113
8 0.0125698
5 0.00127046
3 0.128668
2 0.0206026
EOD
$px_per_period_accurate << EOD
32 4.35466
16 0.0124113
8 0.0125698
5 0.00127046
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
10 0.00702287
40 0.0117421
70 0.0100193
100 0.00386096
120 0.373155
EOD
$phase_angle_accurate << EOD
10 0.00702287
40 0.0117421
70 0.0100193
100 0.00386096
120 0.351131
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
0 0.00769408
1 0.272984
2 0.275016
3 0.323482
4 0.284254
5 0.941725
EOD
$tilt_accurate << EOD
0 0.00769408
1 0.272984
2 0.275016
3 0.323482
4 0.307587
5 0.927529
EOD
$exposure_fast << EOD
1 0.952729
10 1.38869
EOD
$exposure_balanced << EOD
1 0.00769408
10 0.0128998
30 0.032556
300 0.189151
EOD
$exposure_accurate << EOD
1 0.00769408
10 0.0128998
30 0.032556
300 0.189151
EOD
set terminal pngcairo size 1900,850 font ',10'
set output '/tmp/w2/sweep/sweep_error.png'
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
set output '/tmp/w2/sweep/sweep_error.svg'
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
