$$ A rational NURBS weight cannot be represented.
GOTO/0,0,0
NURBS/
KNOT/1.0
CNTRL/1,1,0,0.5
CNTRL/2,0,0
GOTO/3,0,0
