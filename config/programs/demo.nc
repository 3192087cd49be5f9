%demo
( liftd demo: a small nesting job on a flatbed laser cutter.                   )
( Z cuts 1 mm above the sheet. Between parts the laser is off and Z lifts      )
( automatically; with Advanced Lifting it rises as high as its dynamics allow  )
( and is back at 1 mm, at rest, exactly when XY reaches the next pierce point. )
N10 G90 G17 G94
#SLOPE[TYPE=TRAPEZ]
N20 G00 X20 Y20 Z1
( part 1: plate 160 x 100 with two rounded corners )
N30 M04                                     ; laser on: waits for the PLC (pierce)
N40 G01 X180 Y20 F6000
N50 X180 Y100
N60 G03 X160 Y120 I-20 J0
N70 G01 X40 Y120
N80 G03 X20 Y100 I0 J-20
N90 G01 X20 Y20
N100 M05                                    ; laser off
( travel to part 2: cross-block lift over two blocks )
N110 Z[LIFT_START POS=1 POS_LIMIT=60]
N120 G01 X260 Y60 F24000
N130 X300 Y70
N140 Z[LIFT_END]
( part 2: full circle R30 )
N150 M04
N160 G02 I30 J0 F5000
N170 M05
( travel to part 3 in one block: single-block lift )
N180 G01 X420 Y40 F24000 Z[LIFT POS=1 POS_LIMIT=40]
( part 3: slot with semicircular ends )
N190 M04
N200 G01 X520 Y40 F6000
N210 G03 X520 Y80 R20
N220 G01 X420 Y80
N230 G03 X420 Y40 R20
N240 M05
( travel to part 4 )
N250 Z[LIFT_START POS=1 POS_LIMIT=60]
N260 G01 X440 Y110 F24000
N270 X460 Y150
N280 Z[LIFT_END]
( part 4: square 20 x 20 cut in two passes around a 4 mm micro-joint )
N290 M04
N300 G01 X480 Y150 F6000
N310 Y170
N320 X476
N330 M05
( the hop over the micro-joint is shorter than lift_min_dist (5 mm): suppressed )
N340 Z[LIFT_START POS=1 POS_LIMIT=40]
N350 G01 X472 F24000
N360 Z[LIFT_END]
N370 M04
N380 G01 X460 F6000
N390 Y150
N400 M05
( park: lift to a new target height on the way back )
N410 Z[LIFT_START POS=50 POS_LIMIT=80]
N420 G00 X20 Y20
N430 Z[LIFT_END]
N440 M30
