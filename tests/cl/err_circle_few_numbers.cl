$$ CIRCLE needs at least the centre and the axis (6 numbers).
GOTO/10,0,0
CIRCLE/0,0,0,0,0
GOTO/0,10,0
