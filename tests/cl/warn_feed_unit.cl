$$ A metric file whose FEDRAT says inches per minute.
UNITS/MM
FEDRAT/IPM,10
GOTO/1,2,3
FEDRAT/IPM,20
GOTO/4,5,6
