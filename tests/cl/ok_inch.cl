$$ An inch file: coordinates and feeds are converted to mm.
UNITS/INCHES
FEDRAT/IPM,10
GOTO/1,2,3
GOTO/1,2,3,0,0,1
