$$ The end point of the arc is 1 mm off the circle of radius 10.
GOTO/10,0,0
CIRCLE/0,0,0,0,0,1,10
GOTO/0,11,0
