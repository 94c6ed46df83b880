# window.gp: written by tools/convergence_report.py; gnuplot window.gp (in this folder) redraws window.png
set terminal pngcairo size 900,720 font ",11"
set output "window.png"
set datafile separator ","
set logscale xy
set grid xtics ytics mxtics mytics lc rgb '#dddddd'
set xlabel "seconds (rendering time, photon passes and map building included)"
set ylabel "relMSE against the reference"
set title "scenes/window-room.gltf: relMSE against time, 64x64"
set key outside below maxrows 6 font ',9'
set xrange [0.05:41.6]
plot 'data/window-ppm-a0.67-gather.csv' every ::1 using 1:5 with lines lc rgb "#2ca02c" lw 2 dt 1 title 'PPM a=2/3, indirect gather', \
     'data/window-ppm-unguided.csv' every ::1 using 1:5 with lines lc rgb "#bcbd22" lw 2 dt 1 title 'PPM a=2/3, gather, photons not guided (--guide off)', \
     'data/window-ppm-unclipped-unguided.csv' every ::1 using 1:5 with lines lc rgb "#7f7f7f" lw 2 dt 1 title 'PPM a=2/3, gather, estimates unclipped, photons not guided (--clip off --guide off)', \
     'data/window-pt.csv' every ::1 using 1:5 with lines lc rgb "#000000" lw 3 dt 1 title 'path tracing', \
     0.0165197*x**-1 with lines lc rgb '#aaaaaa' dt 2 title 'slope -1', \
     0.0165197*x**(-2./3) with lines lc rgb '#aaaaaa' dt 3 title 'slope -2/3'
