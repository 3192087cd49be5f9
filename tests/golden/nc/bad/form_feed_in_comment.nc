; expect 990018 line 6
N10 G90 G17 G94 G00 X20 Y20 Z1 (part 1page 2 of the printout)
()
N20 G01 X100 F6000

N30 G01 X150 Q1
N99 M30
