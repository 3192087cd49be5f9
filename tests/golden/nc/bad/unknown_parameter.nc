; expect 20925 line 2
G01 X[P12+10] F6000
M30
