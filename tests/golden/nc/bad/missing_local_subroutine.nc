; expect 990020 line 3
G01 X10 Y10 F6000
LL not_defined
M30
