; expect 21542 line 6
%L hole
G02 I5 J0 F3000
M17
%main
G00 X20 Y20 LL hole X30
M30
