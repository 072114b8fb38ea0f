$$ A peck-drilling cycle without its peck depth.
GOTO/0,0,25
CYCLE/DEEP,DEPTH,20,MMPM,100,CLEAR,2
GOTO/0,0,0
CYCLE/OFF
