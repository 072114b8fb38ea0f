$$ The first CIRCLE lost its end-point GOTO: another CIRCLE follows it.
GOTO/10,0,0
CIRCLE/0,0,0,0,0,1,10
CIRCLE/0,0,0,0,0,1,10
GOTO/0,10,0
