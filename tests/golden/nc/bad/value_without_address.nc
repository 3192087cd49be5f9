; expect 990001 line 4
N10 G90 G17 G94 G00 X20 Y20 Z1
N20 G01 X100 F6000
N30 G01 X150 20 (the Y of this block lost its letter)
N99 M30
