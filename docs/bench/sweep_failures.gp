$max_slope_fast << EOD
0.01 0
0.02 0
0.04 0
0.08 0
0.16 0
0.24 0
0.4 0
EOD
$max_slope_balanced << EOD
0.01 0
0.02 0
0.04 0
0.08 0
0.16 0
0.24 0
0.4 0
EOD
$max_slope_accurate << EOD
0.01 0
0.02 0
0.04 0
0.08 0
0.16 0
0.24 0
0.4 0
EOD
$noise_fast << EOD
200000 0
20000 0
5000 0
2000 0
800 0
300 0
EOD
$noise_balanced << EOD
200000 0
20000 0
5000 0
2000 0
800 0
300 0
EOD
$noise_accurate << EOD
200000 0
20000 0
5000 0
2000 0
800 0
300 0
EOD
$blur_fast << EOD
0.3 0
0.6 0
1.2 0
2.4 0
4 0
6 0
EOD
$blur_balanced << EOD
0.3 0
0.6 0
1.2 0
2.4 0
4 0
6 0
EOD
$blur_accurate << EOD
0.3 0
0.6 0
1.2 0
2.4 0
4 0
6 0
EOD
$px_per_period_fast << EOD
32 0
16 0
8 0
5 0
3 0
2 0
EOD
$px_per_period_balanced << EOD
32 0
16 0
8 0
5 0
3 0
2 0
EOD
$px_per_period_accurate << EOD
32 0
16 0
8 0
5 0
3 0
2 0
EOD
$phase_angle_fast << EOD
10 0
40 0
70 0
100 0
120 0
140 1
EOD
$phase_angle_balanced << EOD
10 0
40 0
70 0
100 0
120 0
140 1
EOD
$phase_angle_accurate << EOD
10 0
40 0
70 0
100 0
120 0
140 1
EOD
$tilt_fast << EOD
0 0
1 0
2 0
3 0
4 0
5 0
EOD
$tilt_balanced << EOD
0 0
1 0
2 0
3 0
4 0
5 0
EOD
$tilt_accurate << EOD
0 0
1 0
2 0
3 0
4 0
5 0
EOD
$exposure_fast << EOD
1 0
10 0
30 1
100 1
300 1
EOD
$exposure_balanced << EOD
1 0
10 0
30 0.333333
100 1
300 1
EOD
$exposure_accurate << EOD
1 0
10 0
30 0.333333
100 1
300 1
EOD
$stray_light_fast << EOD
0 0
0.01 0
0.02 0
0.04 0
0.08 0
0.16 0
EOD
$stray_light_balanced << EOD
0 0
0.01 0
0.02 0
0.04 0
0.08 0
0.16 0
EOD
$stray_light_accurate << EOD
0 0
0.01 0
0.02 0
0.04 0
0.08 0
0.16 0
EOD
set terminal pngcairo size 1900,850 font ',10'
set output 'docs/bench/sweep_failures.png'
set multiplot layout 2,4 title 'weavefit stability: share of wrong (model, or > 3 stated errors off) or unresolved answers (a sinusoid, m 0.24, 1.44 mm = 16 px per period, 320x240, alpha 30 deg; one axis varied at a time)'
set grid
set key top left
set logscale x
unset logscale y
set yrange [-0.05:1.05]
set xlabel 'max slope m'
plot $max_slope_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $max_slope_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $max_slope_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
set logscale x
unset logscale y
set yrange [-0.05:1.05]
set xlabel 'photons at full scale (fewer = noisier)'
plot $noise_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $noise_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $noise_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
set logscale x
unset logscale y
set yrange [-0.05:1.05]
set xlabel 'source blur sigma, deg'
plot $blur_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $blur_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $blur_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
set logscale x
unset logscale y
set yrange [-0.05:1.05]
set xlabel 'pixels per thread period'
plot $px_per_period_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $px_per_period_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $px_per_period_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
unset logscale x
unset logscale y
set yrange [-0.05:1.05]
set xlabel 'phase angle, deg'
plot $phase_angle_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $phase_angle_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $phase_angle_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
unset logscale x
unset logscale y
set yrange [-0.05:1.05]
set xlabel 'axis tilt, deg'
plot $tilt_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $tilt_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $tilt_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
set logscale x
unset logscale y
set yrange [-0.05:1.05]
set xlabel 'exposure, times the default (glints clip)'
plot $exposure_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $exposure_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $exposure_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
unset logscale x
unset logscale y
set yrange [-0.05:1.05]
set xlabel 'stray light, full-scale level of a lit crest'
plot $stray_light_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $stray_light_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $stray_light_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
unset multiplot
set terminal svg size 1900,850
set output 'docs/bench/sweep_failures.svg'
set multiplot layout 2,4 title 'weavefit stability: share of wrong (model, or > 3 stated errors off) or unresolved answers (a sinusoid, m 0.24, 1.44 mm = 16 px per period, 320x240, alpha 30 deg; one axis varied at a time)'
set grid
set key top left
set logscale x
unset logscale y
set yrange [-0.05:1.05]
set xlabel 'max slope m'
plot $max_slope_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $max_slope_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $max_slope_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
set logscale x
unset logscale y
set yrange [-0.05:1.05]
set xlabel 'photons at full scale (fewer = noisier)'
plot $noise_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $noise_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $noise_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
set logscale x
unset logscale y
set yrange [-0.05:1.05]
set xlabel 'source blur sigma, deg'
plot $blur_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $blur_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $blur_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
set logscale x
unset logscale y
set yrange [-0.05:1.05]
set xlabel 'pixels per thread period'
plot $px_per_period_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $px_per_period_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $px_per_period_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
unset logscale x
unset logscale y
set yrange [-0.05:1.05]
set xlabel 'phase angle, deg'
plot $phase_angle_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $phase_angle_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $phase_angle_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
unset logscale x
unset logscale y
set yrange [-0.05:1.05]
set xlabel 'axis tilt, deg'
plot $tilt_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $tilt_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $tilt_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
set logscale x
unset logscale y
set yrange [-0.05:1.05]
set xlabel 'exposure, times the default (glints clip)'
plot $exposure_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $exposure_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $exposure_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
unset logscale x
unset logscale y
set yrange [-0.05:1.05]
set xlabel 'stray light, full-scale level of a lit crest'
plot $stray_light_fast using 1:2 with linespoints lw 2 pt 5 title 'peak picking (fast)', $stray_light_balanced using 1:2 with linespoints lw 2 pt 7 title 'lobe fit + glints (balanced)', $stray_light_accurate using 1:2 with linespoints lw 2 pt 9 title 'lobe fits from 2 starts + glints (accurate)'
unset multiplot
