$$ A GOTO whose tool axis is the zero vector.
GOTO/1,2,3,0,0,0
