$$ Vendor words the reader does not know (CATIA peening PP table).
GOTO/1,2,3
GOHOME
SPINDLE/CLW20
GOHOME
