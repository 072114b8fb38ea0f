$$ A cycle word the reader does not know (Creo web drilling).
GOTO/0,0,25
CYCLE/THRU,DEPTH,5,MMPM,100,CLEAR,2
GOTO/0,0,0
CYCLE/OFF
