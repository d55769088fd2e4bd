$max_slope_fast << EOD
0.02 0.0458964
0.04 0.246595
0.08 0.787385
0.16 0.621814
0.24 0.953566
0.4 0.425517
EOD
$max_slope_balanced << EOD
0.02 0.0458964
0.04 0.246595
0.08 0.00220472
0.16 0.00320244
0.24 0.0116702
0.4 0.0216905
EOD
$max_slope_accurate << EOD
0.02 0.0458964
0.04 0.246595
0.08 0.00220472
0.16 0.00320244
0.24 0.0116702
0.4 0.0216905
EOD
$noise_fast << EOD
200000 0.927452
20000 0.953566
5000 0.910298
2000 0.803555
800 0.838996
300 0.780592
EOD
$noise_balanced << EOD
200000 0.00399382
20000 0.0116702
5000 0.0160811
2000 0.0173519
800 0.813304
300 0.870367
EOD
$noise_accurate << EOD
200000 0.00399382
20000 0.0116702
5000 0.0160811
2000 0.0173519
800 0.813304
300 0.870367
EOD
$blur_fast << EOD
0.3 1.25078
0.6 0.953566
1.2 0.424615
2.4 0.56742
4 1.44191
6 2.76761
EOD
$blur_balanced << EOD
0.3 0.0182374
0.6 0.0116702
1.2 0.00940709
2.4 0.00859407
4 0.052408
6 0.0628387
EOD
$blur_accurate << EOD
0.3 0.0182374
0.6 0.0116702
1.2 0.00940709
2.4 0.00859407
4 0.052408
6 0.0628387
EOD
$px_per_period_fast << EOD
32 4.35493
16 3.18404
8 0.972056
5 0.14609
3 0.131617
2 0.0220121
EOD
$px_per_period_balanced << EOD
32 4.35493
16 0.0103667
8 0.00483825
5 0.00690512
3 0.0592855
2 0.0513899
EOD
$px_per_period_accurate << EOD
32 4.35493
16 0.0103667
8 0.00483825
5 0.00690512
3 0.0592855
2 0.0513899
EOD
$phase_angle_fast << EOD
10 0.23899
40 0.174364
70 0.655388
100 0.592448
120 0.709471
EOD
$phase_angle_balanced << EOD
10 0.00117198
40 0.0111537
70 0.00774105
100 0.0076613
120 0.358379
EOD
$phase_angle_accurate << EOD
10 0.00117198
40 0.0111537
70 0.00774105
100 0.0076613
120 0.358379
EOD
$tilt_fast << EOD
0 0.953566
1 0.978239
2 0.887923
3 0.962049
4 0.962098
5 0.943227
EOD
$tilt_balanced << EOD
0 0.0116702
1 0.265526
2 0.261624
3 0.32611
4 0.908931
5 0.919059
EOD
$tilt_accurate << EOD
0 0.0116702
1 0.265526
2 0.261624
3 0.32611
4 0.908931
5 0.919059
EOD
$exposure_fast << EOD
1 0.953566
10 1.40897
EOD
$exposure_balanced << EOD
1 0.0116702
10 0.0178054
30 0.0406516
EOD
$exposure_accurate << EOD
1 0.0116702
10 0.0178054
30 0.0406516
EOD
$stray_light_fast << EOD
0 0.953566
0.01 0.936301
0.02 0.966292
0.04 0.972708
0.08 1.15191
0.16 1.64032
EOD
$stray_light_balanced << EOD
0 0.0116702
0.01 0.00742257
0.02 0.0094123
0.04 0.0200405
0.08 0.0439822
0.16 0.953402
EOD
$stray_light_accurate << EOD
0 0.0116702
0.01 0.00742257
0.02 0.0094123
0.04 0.0200405
0.08 0.0439822
0.16 0.985709
EOD
set terminal pngcairo size 1900,850 font ',10'
set output 'docs/bench/sweep_error.png'
set multiplot layout 2,4 title 'weavefit stability: median |peak spacing error|, deg (a sinusoid, m 0.24, 1.44 mm = 16 px per period, 320x240, alpha 30 deg; one axis varied at a time)'
set grid
set key top left
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'max slope m'
plot $max_slope_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $max_slope_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $max_slope_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'photons at full scale (fewer = noisier)'
plot $noise_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $noise_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $noise_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'source blur sigma, deg'
plot $blur_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $blur_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $blur_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'pixels per thread period'
plot $px_per_period_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $px_per_period_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $px_per_period_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
unset logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'phase angle, deg'
plot $phase_angle_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $phase_angle_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $phase_angle_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
unset logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'axis tilt, deg'
plot $tilt_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $tilt_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $tilt_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'exposure, times the default (glints clip)'
plot $exposure_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $exposure_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $exposure_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
unset logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'stray light, full-scale level of a lit crest'
plot $stray_light_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $stray_light_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $stray_light_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
unset multiplot
set terminal svg size 1900,850
set output 'docs/bench/sweep_error.svg'
set multiplot layout 2,4 title 'weavefit stability: median |peak spacing error|, deg (a sinusoid, m 0.24, 1.44 mm = 16 px per period, 320x240, alpha 30 deg; one axis varied at a time)'
set grid
set key top left
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'max slope m'
plot $max_slope_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $max_slope_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $max_slope_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'photons at full scale (fewer = noisier)'
plot $noise_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $noise_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $noise_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'source blur sigma, deg'
plot $blur_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $blur_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $blur_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'pixels per thread period'
plot $px_per_period_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $px_per_period_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $px_per_period_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
unset logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'phase angle, deg'
plot $phase_angle_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $phase_angle_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $phase_angle_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
unset logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'axis tilt, deg'
plot $tilt_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $tilt_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $tilt_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
set logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'exposure, times the default (glints clip)'
plot $exposure_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $exposure_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $exposure_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
unset logscale x
set logscale y
set yrange [0.0005:30]
set xlabel 'stray light, full-scale level of a lit crest'
plot $stray_light_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $stray_light_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $stray_light_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
unset multiplot
