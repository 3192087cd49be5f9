( US SHOP PROGRAM - dimensions in inch (G70), feeds in inch/min                     )
( the operator shifts the part origin with G92 instead of a zero offset             )
%inch
N10 G90 G17 G70 G94
N20 #SLOPE[TYPE=TRAPEZ]
N30 G00 X1 Y1 Z0.04
N40 G92 X2 Y2                           ( reference point offset: part origin at 2/2 inch )
N50 G00 X0 Y0
N60 M04
N70 G01 X4 F240                         ( 240 inch/min = 101.6 mm/s )
N80 Y2
N90 G03 X3 Y3 R1
N100 G01 X0
N110 Y0
N120 M05
N130 Z[LIFT_START G91 POS=0 POS_LIMIT=1.5]  ( POS and POS_LIMIT relative, in inch )
N140 G01 X8 F900
N150 Y1
N160 Z[LIFT_END]
N170 M04
N180 G02 I0.5 J0 F200
N190 M05
N200 G92 X0 Y0
N210 G71 Z[LIFT_START POS=1 POS_LIMIT=60]
N220 G00 X0 Y0
N230 Z[LIFT_END]
N240 M30
