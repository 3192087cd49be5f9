( the small program of issue 19 as a nesting CAM writes it: a local subroutine with a   )
( pierce and a full circle, HSC on for the job, technology H word, kerf-compensated     )
( contour, a lift to the next part and the subroutine call                              )
%L part_hole
N1 G00 X[P1] Y[P2]
N2 M04
N3 G02 I5 J0 F3000
N4 M05
N5 M17
%nest_0815
N10 G90 G17 G71 G94
N20 #HSC ON [OPMODE 2 PATH_DEV 0.05]
N30 H10 D1
N40 G54
N50 G00 X10 Y10 Z1
N60 M04
N70 G41 G01 X20 Y10 F6000
N80 X60
N90 Y40
N100 X20
N110 Y10
N120 G40 X15 Y5
N130 M05
N140 Z[LIFT_START POS=1 POS_LIMIT=60]
N150 G00 X90 Y20
N160 Z[LIFT_END]
N170 P1=100 P2=20
N180 LL part_hole
N190 M30
