$$ The first CIRCLE lost its end-point GOTO: another CIRCLE follows it. (The lead-in along +Y
$$ is tangent to the second arc: its sense is counter-clockwise.)
GOTO/10,-5,0
GOTO/10,0,0
CIRCLE/0,0,0,0,0,1,10
CIRCLE/0,0,0,0,0,1,10
GOTO/0,10,0
