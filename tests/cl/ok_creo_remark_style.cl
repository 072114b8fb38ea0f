PARTNO / MFG0001
REMARK *          PRO/CLFILE  VERSION 9.0 - 9.0.3.0
REMARK -> FEATNO / 1014
UNITS / MM
$$ Creo's REMARK output style: the header and the operation marker are REMARKs, not APT source.
RAPID 
GOTO / 1.0000000000, 2.0000000000, 3.0000000000
REMARK -> END /
FINI 
