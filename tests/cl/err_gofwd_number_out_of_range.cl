$$ CATIA APT motion whose circle radius is out of range (`2.E40000` is infinite).
GOTO/30.4,0,-2
INDIRV/0,0,1
TLON,GOFWD/(CIRCLE/28,0,-2,2.E40000),ON,(LINE/28,0,-2,28,0,0.4)
