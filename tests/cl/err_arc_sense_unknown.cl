$$ No CAM system recognised and no move tangent to the arc: its sense is unknown.
FEDRAT/1000
GOTO/10,0,10
GOTO/10,0,0
CIRCLE/0,0,0,0,0,1,10
GOTO/0,10,0
GOTO/0,10,10
