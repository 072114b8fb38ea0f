$$ A CATIA lathe program: a turret index and a turning tool, feeds per revolution.
TURRET/1,OSETNO,1,SETOOL,0,0,0
TOOLNO/1,TURN,1,0,3,0.4,0,0,0.1,MMPR,500,SFM,CCLW,ON,0,NOTE
FEDRAT/0.1,MMPR
SPINDL/500,SFM,CCLW
GOTO/17,0,2
GOTO/17,0,0
