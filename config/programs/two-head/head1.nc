%head1
( liftd two-head demo, channel 1: head 1 (X Y Z) cuts the left sheet.      )
( Advanced Lifting: Z rises as high as its dynamics allow between parts.   )
N10 G90 G17 G94
#SLOPE[TYPE=TRAPEZ]
N20 G00 X20 Y20 Z1
( part 1: plate 160 x 100 with two rounded corners )
N30 M04
N40 G01 X180 Y20 F6000
N50 X180 Y100
N60 G03 X160 Y120 I-20 J0
N70 G01 X40 Y120
N80 G03 X20 Y100 I0 J-20
N90 G01 X20 Y20
N100 M05
( travel to part 2 over two blocks )
N110 Z[LIFT_START POS=1 POS_LIMIT=60]
N120 G01 X260 Y60 F24000
N130 X300 Y70
N140 Z[LIFT_END]
( part 2: full circle R30 )
N150 M04
N160 G02 I30 J0 F5000
N170 M05
( travel to part 3 in one block )
N180 G01 X420 Y40 F24000 Z[LIFT POS=1 POS_LIMIT=40]
( part 3: slot with semicircular ends )
N190 M04
N200 G01 X520 Y40 F6000
N210 G03 X520 Y80 R20
N220 G01 X420 Y80
N230 G03 X420 Y40 R20
N240 M05
( park )
N250 Z[LIFT_START POS=50 POS_LIMIT=80]
N260 G00 X20 Y20
N270 Z[LIFT_END]
N280 M30
