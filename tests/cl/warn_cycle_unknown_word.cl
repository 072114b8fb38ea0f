$$ A cycle keyword the reader does not know: ignored, kept in the cycle's text.
GOTO/0,0,25
CYCLE/DRILL,DEPTH,5,MMPM,100,CLEAR,2,SPEED,3
GOTO/0,0,0
CYCLE/OFF
