# written by bench/rsf_kc_map (data: rsf_kc_map.dat)
set terminal pngcairo size 1150,480 font ',10'
set output 'rsf_kc_map.png'
set multiplot layout 1,2 title 'Rate-and-state spring-slider: stick-slip amplitude (max - min F_d over the last 30 %) / (F_N mu_{ss}(V)), from rest'
set logscale y
set format y '10^{%L}'
set xrange [0.475:1.525]
set yrange [7e-6:7e-3]
set xlabel 'k_d / k_c(V),   k_c = F_N (b - a)/D_c (1 + m V^2/(F_N a D_c))'
set ylabel 'drive velocity V [m/s]'
set cbrange [0:1.2]
set palette defined (0 'white', 0.05 '#ffffcc', 0.4 '#fd8d3c', 1.2 '#800026')
set style fill solid noborder
set arrow 1 from 1,7e-6 to 1,7e-3 nohead lc 'black' lw 2 front
set key bottom left box opaque
set title 'aging law'
unset colorbox
plot 'rsf_kc_map.dat' index 0 using 3:2:($3-0.025):($3+0.025):($2/1.41):($2*1.41):4 with boxxyerror fc palette notitle, 'rsf_kc_map.dat' index 2 using 1:2 with lines dt 2 lw 2 lc 'black' title 'quasi-static k_c', 1/0 with lines lw 2 lc 'black' title 'k_c(V)'
set title 'slip law'
set cblabel 'amplitude / steady friction'
set colorbox
plot 'rsf_kc_map.dat' index 1 using 3:2:($3-0.025):($3+0.025):($2/1.41):($2*1.41):4 with boxxyerror fc palette notitle, 'rsf_kc_map.dat' index 2 using 1:2 with lines dt 2 lw 2 lc 'black' title 'quasi-static k_c', 1/0 with lines lw 2 lc 'black' title 'k_c(V)'
unset multiplot
