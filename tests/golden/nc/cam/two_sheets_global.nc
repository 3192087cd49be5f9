( TWO SHEETS - 4 flanges D80 each - sheet origins G54 / G55 from the zero-offset list )
( global subroutine per part (L lib/flange_d80.nc), gas on with M08 per sheet        )
%two_sheets
N10 G90 G17 G71 G94
N20 #SLOPE[TYPE=TRAPEZ]
N30 D1
N40 G54
N50 G00 X0 Y0 Z1
N60 M08
N70 P1=60 P2=60
N80 L lib/flange_d80.nc
N90 P1=160
N100 L lib/flange_d80.nc
N110 P2=160
N120 L lib/flange_d80.nc
N130 P1=60
N140 L lib/flange_d80.nc
( second sheet: same parts, other origin )
N200 Z[LIFT_START POS=1 POS_LIMIT=100]
N210 G55 G00 X0 Y0
N220 Z[LIFT_END]
N230 P1=60 P2=60
N240 L lib/flange_d80.nc
N250 P1=160
N260 L lib/flange_d80.nc
N900 Z[LIFT_START POS=1 POS_LIMIT=80]
N910 G53 G00 X0 Y0
N920 Z[LIFT_END]
N930 M30
