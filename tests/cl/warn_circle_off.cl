$$ The end point of the arc is 1 mm off the circle of radius 10. (The lead-in along +Y is
$$ tangent to the arc: its sense is counter-clockwise.)
GOTO/10,-5,0
GOTO/10,0,0
CIRCLE/0,0,0,0,0,1,10
GOTO/0,11,0
