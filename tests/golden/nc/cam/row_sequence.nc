( ROW OF 8 SMALL PLATES 30 x 15 - geometry already kerf-compensated by the CAM      )
( one row programmed once and repeated with L SEQUENCE; single-block lifts; G261     )
( polynomial contouring is switched on by the post-processor (runs unsmoothed here)  )
%row
N10 G90 G17 G71 G94
N20 #SLOPE[TYPE=TRAPEZ]
N30 G54 G00 X0 Y0 Z1
N40 P1=10 P2=10
N50 G261
N100 G01 X[P1] Y[P2] F24000 Z[LIFT POS=1 POS_LIMIT=30]
N110 M04
N120 G91 G01 X30 F6000
N130 Y15
N140 X-30
N150 Y-15
N160 G90
N170 M05
N180 P1=P1+40
N190 L SEQUENCE [N100 N180 REPEAT=7]
N200 G260
N210 G01 X0 Y0 F24000 Z[LIFT POS=60 POS_LIMIT=60]
N220 M30
