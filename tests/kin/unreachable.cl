$$ The tool axis points down at line 6: no Mikron UCP 710 solution (A would be 180 deg).
UNITS/MM
FEDRAT/MMPM,1000
GOTO/0,0,10,0,0,1
GOTO/0,0,5,0,0,1
GOTO/0,0,0,0,0,-1
FINI
