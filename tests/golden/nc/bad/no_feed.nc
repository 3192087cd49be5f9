; expect 20008 line 2
N10 G01 X10 Y10
