$$ APT-source motion that cannot be evaluated: the CIRCLE has 3 values, not cx,cy,cz,r.
GOTO/25,0,-25.4
INDIRV/0,0,1
TLON,GOFWD/(CIRCLE/1,2,3),ON,(LINE/1,2,3,4,5,6)
