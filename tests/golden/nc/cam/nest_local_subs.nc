( NESTING JOB 0815 - sheet 1500 x 1000 x 3 mm S235 - laser 4 kW N2               )
( post-processor: ISG laser, one local subroutine per part shape, kerf by G42/D1 )
( part origin in P1/P2 (lower left), lifts between the parts                      )
%L bracket_60x30
( outer contour counter-clockwise, tool right = outside; lead-in from the left )
N1 M04                                  ( pierce, waits for the PLC )
N2 G42 G01 X[P1] Y[P2+15] F6000
N3 Y[P2]
N4 X[P1+60]
N5 Y[P2+22]
N6 G03 X[P1+52] Y[P2+30] I-8 J0         ( rounded corner R8 )
N7 G01 X[P1]
N8 Y[P2+15]
N9 G40 X[P1-2] Y[P2+15]
N10 M05
N11 M17
%L hole_d10
( hole: pierce in the centre P3/P4, radial lead-in, clockwise, tool right = inside )
N20 M04
N21 G42 G01 X[P3+5] Y[P4] F3000
N22 G02 I-5 J0
N23 G40 G01 X[P3] Y[P4]
N24 M05
N25 M29
%nest_0815
N100 G90 G17 G71 G94
N110 #SLOPE[TYPE=TRAPEZ]
N120 #HSC ON [OPMODE 2 PATH_DEV 0.05]    ( the CAM switches HSC on for the whole job )
N130 H10 D1                             ( technology table 10, kerf tool 1 )
N140 G54                                ( sheet origin )
N150 G00 X0 Y0 Z1
( part 1 at X20 Y20: holes first, then the contour )
N200 P1=20 P2=20 P3=P1+15 P4=P2+15
N210 G00 X[P3] Y[P4]
N220 LL hole_d10
N230 Z[LIFT_START POS=1 POS_LIMIT=40]
N240 G00 X[P1-2] Y[P2+15]
N250 Z[LIFT_END]
N260 LL bracket_60x30
( part 2 at X100 Y20 )
N300 P1=100 P3=P1+15
N310 Z[LIFT_START POS=1 POS_LIMIT=40]
N320 G00 X[P3] Y[P4]
N330 Z[LIFT_END]
N340 LL hole_d10
N350 Z[LIFT_START POS=1 POS_LIMIT=40]
N360 G00 X[P1-2] Y[P2+15]
N370 Z[LIFT_END]
N380 LL bracket_60x30
( part 3 at X100 Y70, rotated copy is not needed: same shape )
N400 P2=70 P4=P2+15
N410 Z[LIFT_START POS=1 POS_LIMIT=40]
N420 G00 X[P3] Y[P4]
N430 Z[LIFT_END]
N440 LL hole_d10
N450 Z[LIFT_START POS=1 POS_LIMIT=40]
N460 G00 X[P1-2] Y[P2+15]
N470 Z[LIFT_END]
N480 LL bracket_60x30
N900 Z[LIFT_START POS=80 POS_LIMIT=80]   ( park )
N910 G00 X0 Y0
N920 Z[LIFT_END]
N930 #HSC OFF
N940 M30
