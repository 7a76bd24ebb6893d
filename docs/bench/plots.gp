set terminal pngcairo size 800,520
set grid
set key top left
set output 'time_vs_motion.png'
set title 'Raytrace cost grows with head translation (003 eq. 11)'
set xlabel 'head translation, cm'
set ylabel 'ms per frame, both eyes'
plot 'time_vs_motion.dat' u 1:2 w lp lw 2 t 'raytrace + lens', '' u 1:3 w lp lw 2 t 'rotation + lens', '' u 1:5 w lp lw 2 t 'raytrace at the mesh vertices'
set output 'quality_vs_time_room.png'
set title 'Scene room, 8 deg + 5 cm: quality vs time'
set xlabel 'ms per frame, one eye, single thread (log)'
set ylabel 'PSNR vs ground truth, dB'
set logscale x
plot 'sweep_room.dat' index 0 u 1:2 w p pt 7 ps 1.3 t 'configurations', '' index 0 u 1:2:3 w labels offset 0,1 font ',7' notitle, '' index 1 u 1:2 w lp lw 2 lc rgb 'red' t 'Pareto front'
unset logscale x
set output 'quality_vs_time_near.png'
set title 'Scene near, 8 deg + 5 cm: quality vs time'
set xlabel 'ms per frame, one eye, single thread (log)'
set ylabel 'PSNR vs ground truth, dB'
set logscale x
plot 'sweep_near.dat' index 0 u 1:2 w p pt 7 ps 1.3 t 'configurations', '' index 0 u 1:2:3 w labels offset 0,1 font ',7' notitle, '' index 1 u 1:2 w lp lw 2 lc rgb 'red' t 'Pareto front'
unset logscale x
set output 'quality_vs_time_hairball.png'
set title 'Scene hairball, 8 deg + 5 cm: quality vs time'
set xlabel 'ms per frame, one eye, single thread (log)'
set ylabel 'PSNR vs ground truth, dB'
set logscale x
plot 'sweep_hairball.dat' index 0 u 1:2 w p pt 7 ps 1.3 t 'configurations', '' index 0 u 1:2:3 w labels offset 0,1 font ',7' notitle, '' index 1 u 1:2 w lp lw 2 lc rgb 'red' t 'Pareto front'
unset logscale x
set output 'quality_vs_time_glass.png'
set title 'Scene glass, 8 deg + 5 cm: quality vs time'
set xlabel 'ms per frame, one eye, single thread (log)'
set ylabel 'PSNR vs ground truth, dB'
set logscale x
plot 'sweep_glass.dat' index 0 u 1:2 w p pt 7 ps 1.3 t 'configurations', '' index 0 u 1:2:3 w labels offset 0,1 font ',7' notitle, '' index 1 u 1:2 w lp lw 2 lc rgb 'red' t 'Pareto front'
unset logscale x
set output 'quality_vs_time_movers.png'
set title 'Scene movers, 8 deg + 5 cm: quality vs time'
set xlabel 'ms per frame, one eye, single thread (log)'
set ylabel 'PSNR vs ground truth, dB'
set logscale x
plot 'sweep_movers.dat' index 0 u 1:2 w p pt 7 ps 1.3 t 'configurations', '' index 0 u 1:2:3 w labels offset 0,1 font ',7' notitle, '' index 1 u 1:2 w lp lw 2 lc rgb 'red' t 'Pareto front'
unset logscale x
set output 'quality_vs_time_outdoor.png'
set title 'Scene outdoor, 8 deg + 5 cm: quality vs time'
set xlabel 'ms per frame, one eye, single thread (log)'
set ylabel 'PSNR vs ground truth, dB'
set logscale x
plot 'sweep_outdoor.dat' index 0 u 1:2 w p pt 7 ps 1.3 t 'configurations', '' index 0 u 1:2:3 w labels offset 0,1 font ',7' notitle, '' index 1 u 1:2 w lp lw 2 lc rgb 'red' t 'Pareto front'
unset logscale x
