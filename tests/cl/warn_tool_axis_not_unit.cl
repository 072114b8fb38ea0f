$$ A tool axis of length 2.
GOTO/1,2,3,0,0,2
