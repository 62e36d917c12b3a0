set terminal pngcairo size 920,720 font ',10'
set output 'colas_regime.png'
set multiplot layout 2,2 title 'Measured and predicted stick-slip (karnopp; first stage; labels: regime measured/fitted/held out, S stick-slip, I inertial, C creep)' noenhanced
set logscale x
set xlabel 'k_d [N/m]'
set grid
set key top left font ',8'
set xrange [100:4000]
set ylabel 'median drop [N]'
set title 'v_d = 0.042 mm/s'
unset logscale y
plot 'colas_regime.dat' index 0 using 2:4:5:6 with yerrorbars pt 7 lc rgb 'black' title 'measured (quartiles)', '' index 0 using 2:7 with linespoints pt 4 lc rgb 'blue' title 'fitted', '' index 0 using 2:8 with linespoints pt 6 dt 2 lc rgb 'red' title 'whole run held out', '' index 0 using 2:4:12 with labels offset 2.5,1.0 font ',8' notitle
set ylabel 'median drop [N]'
set title 'v_d = 4.3 mm/s'
unset logscale y
plot 'colas_regime.dat' index 1 using 2:4:5:6 with yerrorbars pt 7 lc rgb 'black' title 'measured (quartiles)', '' index 1 using 2:7 with linespoints pt 4 lc rgb 'blue' title 'fitted', '' index 1 using 2:8 with linespoints pt 6 dt 2 lc rgb 'red' title 'whole run held out', '' index 1 using 2:4:12 with labels offset 2.5,1.0 font ',8' notitle
set ylabel 'drops per second [1/s]'
set title 'v_d = 0.042 mm/s'
set logscale y
plot 'colas_regime.dat' index 0 using 2:9 with points pt 7 lc rgb 'black' title 'measured', '' index 0 using 2:10 with linespoints pt 4 lc rgb 'blue' title 'fitted', '' index 0 using 2:11 with linespoints pt 6 dt 2 lc rgb 'red' title 'whole run held out', '' index 0 using 2:9:12 with labels offset 2.5,1.0 font ',8' notitle
set ylabel 'drops per second [1/s]'
set title 'v_d = 4.3 mm/s'
set logscale y
plot 'colas_regime.dat' index 1 using 2:9 with points pt 7 lc rgb 'black' title 'measured', '' index 1 using 2:10 with linespoints pt 4 lc rgb 'blue' title 'fitted', '' index 1 using 2:11 with linespoints pt 6 dt 2 lc rgb 'red' title 'whole run held out', '' index 1 using 2:9:12 with labels offset 2.5,1.0 font ',8' notitle
unset multiplot
