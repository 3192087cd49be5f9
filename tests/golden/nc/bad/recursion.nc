; expect 20360 line 4
%L again
G91 G01 X0.1 F6000
LL again
M17
%main
G90 G01 X10 Y10 F6000
LL again
M30
