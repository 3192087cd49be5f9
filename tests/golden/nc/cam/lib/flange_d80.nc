( global subroutine: flange D80, 4 bolt holes D8 on PCD 56, centre in P1/P2       )
( called with L lib/flange_d80.nc from the sheet programs; kerf by G41 and the     )
( caller's D word; each travel is a lift range of its own                         )
%L bolt
N1 P6=P1+28*COS[45+P5*90] P7=P2+28*SIN[45+P5*90]
N2 Z[LIFT_START POS=1 POS_LIMIT=25]
N3 G00 X[P6] Y[P7]
N4 Z[LIFT_END]
N5 M04
N6 G41 G01 X[P6+4] Y[P7] F2500          ; radial lead-in, counter-clockwise inside
N7 G03 I-4 J0
N8 G40 G01 X[P6] Y[P7]
N9 M05
N10 P5=P5+1
N11 M17
%flange_d80
N20 P5=0
N30 LL bolt
N40 LL bolt
N50 LL bolt
N60 LL bolt
N70 Z[LIFT_START POS=1 POS_LIMIT=25]
N80 G00 X[P1+48] Y[P2]
N90 Z[LIFT_END]
N100 M04
N110 G41 G01 X[P1+40] Y[P2] F5000      ; outer contour clockwise, tool left = outside
N120 G02 I-40 J0
N130 G40 G01 X[P1+48] Y[P2]
N140 M05
N150 M29
