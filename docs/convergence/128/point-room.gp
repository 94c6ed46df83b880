# point-room.gp: written by tools/convergence_report.py; gnuplot point-room.gp (in this folder) redraws point-room.png
set terminal pngcairo size 900,720 font ",11"
set output "point-room.png"
set datafile separator ","
set logscale xy
set grid xtics ytics mxtics mytics lc rgb '#dddddd'
set xlabel "seconds (rendering time, photon passes and map building included)"
set ylabel "relMSE against the reference"
set title "scenes/point-room.gltf: relMSE against time, 128x128"
set key outside below maxrows 6 font ',9'
set xrange [0.05:31.2]
plot 'data/point-room-default.csv' every ::1 using 1:5 with lines lc rgb "#d62728" lw 3 dt 1 title 'default (no options)', \
     'data/point-room-ppm-photons.csv' every ::1 using 1:5 with lines lc rgb "#2ca02c" lw 2 dt 1 title 'PPM, final gather read from photons (--gather photons)', \
     'data/point-room-ppm-direct.csv' every ::1 using 1:5 with lines lc rgb "#1f77b4" lw 2 dt 2 title 'PPM, photons read at the visible point (--indirect photons)', \
     'data/point-room-classic-1M-gather-disc.csv' every ::1 using 1:5 with lines lc rgb "#8c564b" lw 1.5 dt 3 title 'classic 1M, final gather, disc', \
     'data/point-room-pt.csv' every ::1 using 1:5 with lines lc rgb "#000000" lw 3 dt 1 title 'path tracing', \
     0.0291213*x**-1 with lines lc rgb '#aaaaaa' dt 2 title 'slope -1', \
     0.0291213*x**(-2./3) with lines lc rgb '#aaaaaa' dt 3 title 'slope -2/3'
