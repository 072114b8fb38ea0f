$$ A drilling cycle without its depth (no DEPTH, no FEDTO).
GOTO/0,0,25
CYCLE/DRILL,RAPTO,3.,RTRCTO,25.,MMPM,100.
GOTO/0,0,0
CYCLE/OFF
