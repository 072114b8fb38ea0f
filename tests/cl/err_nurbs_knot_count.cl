$$ A NURBS with 3 control points (the start point included) and 3 knots: degree 0.
GOTO/0,0,0
NURBS/
KNOT/0.5,0.75,1.0
CNTRL/1,1,0
CNTRL/2,0,0
GOTO/3,0,0
