$$ No CAM system recognised: the moves tangent to the arcs decide their sense. The lead-in of
$$ the first arc runs along the clockwise tangent about its axis as written, so the file's arcs
$$ are read clockwise; the second arc has no tangent neighbour and follows the first.
FEDRAT/1000
GOTO/10,5,0
GOTO/10,0,0
CIRCLE/0,0,0,0,0,1,10
GOTO/0,-10,0
GOTO/0,-10,5
GOTO/0,-20,5
CIRCLE/0,-30,5,0,0,1,10
GOTO/10,-30,5
