# caustic.gp: written by tools/convergence_report.py; gnuplot caustic.gp (in this folder) redraws caustic.png
set terminal pngcairo size 900,720 font ",11"
set output "caustic.png"
set datafile separator ","
set logscale xy
set grid xtics ytics mxtics mytics lc rgb '#dddddd'
set xlabel "seconds (rendering time, photon passes and map building included)"
set ylabel "relMSE against the reference"
set title "scenes/caustic.gltf: relMSE against time, 64x64"
set key outside below maxrows 6 font ',9'
set xrange [0.05:83.2]
plot 'data/caustic-ppm-a0.5-gather.csv' every ::1 using 1:5 with lines lc rgb "#1f77b4" lw 2 dt 1 title 'PPM a=1/2, indirect gather', \
     'data/caustic-ppm-a0.67-gather.csv' every ::1 using 1:5 with lines lc rgb "#2ca02c" lw 2 dt 1 title 'PPM a=2/3, indirect gather', \
     'data/caustic-ppm-a0.9-gather.csv' every ::1 using 1:5 with lines lc rgb "#9467bd" lw 2 dt 1 title 'PPM a=0.9, indirect gather', \
     'data/caustic-ppm-a0.5-photons.csv' every ::1 using 1:5 with lines lc rgb "#1f77b4" lw 2 dt 2 title 'PPM a=1/2, indirect photons', \
     'data/caustic-ppm-a0.67-photons.csv' every ::1 using 1:5 with lines lc rgb "#2ca02c" lw 2 dt 2 title 'PPM a=2/3, indirect photons', \
     'data/caustic-ppm-a0.9-photons.csv' every ::1 using 1:5 with lines lc rgb "#9467bd" lw 2 dt 2 title 'PPM a=0.9, indirect photons', \
     'data/caustic-classic-100k-gather-disc.csv' every ::1 using 1:5 with lines lc rgb "#ff7f0e" lw 1.5 dt 3 title 'classic 100k, final gather, disc', \
     'data/caustic-classic-100k-gather-cone.csv' every ::1 using 1:5 with lines lc rgb "#ff7f0e" lw 1.5 dt 4 title 'classic 100k, final gather, cone', \
     'data/caustic-classic-100k-photons-disc.csv' every ::1 using 1:5 with lines lc rgb "#d62728" lw 1.5 dt 3 title 'classic 100k, photons read directly, disc', \
     'data/caustic-classic-100k-photons-cone.csv' every ::1 using 1:5 with lines lc rgb "#d62728" lw 1.5 dt 4 title 'classic 100k, photons read directly, cone', \
     'data/caustic-classic-1M-gather-disc.csv' every ::1 using 1:5 with lines lc rgb "#8c564b" lw 1.5 dt 3 title 'classic 1M, final gather, disc', \
     'data/caustic-classic-1M-gather-cone.csv' every ::1 using 1:5 with lines lc rgb "#8c564b" lw 1.5 dt 4 title 'classic 1M, final gather, cone', \
     'data/caustic-classic-1M-photons-disc.csv' every ::1 using 1:5 with lines lc rgb "#e377c2" lw 1.5 dt 3 title 'classic 1M, photons read directly, disc', \
     'data/caustic-classic-1M-photons-cone.csv' every ::1 using 1:5 with lines lc rgb "#e377c2" lw 1.5 dt 4 title 'classic 1M, photons read directly, cone', \
     'data/caustic-pt.csv' every ::1 using 1:5 with lines lc rgb "#000000" lw 3 dt 1 title 'path tracing', \
     0.179055*x**-1 with lines lc rgb '#aaaaaa' dt 2 title 'slope -1', \
     0.179055*x**(-2./3) with lines lc rgb '#aaaaaa' dt 3 title 'slope -2/3'
