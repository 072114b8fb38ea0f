$$ Siemens NX (TOOL PATH): CIRCLE arcs run clockwise about the axis vector written.
TOOL PATH/CONTOUR,TOOL,MILL-20
FEDRAT/MMPM,1000
GOTO/10,5,0,0,0,1
$$ 1. Axis +Z, 11 values: clockwise seen from +Z, 90 degrees from (10,0,0) to (0,-10,0). The
$$    lead-in runs along -Y, the tangent of a clockwise arc at (10,0,0).
GOTO/10,0,0
CIRCLE/0.0000,0.0000,0.0000,0.0000000,0.0000000,1.0000000,10.0000,0.0600,0.5000,25.0000,0.0000
GOTO/0.0000,-10.0000,0.0000
$$ 2. Axis -Z: clockwise about -Z, counter-clockwise seen from +Z: 90 degrees back to (10,0,0).
CIRCLE/0.0000,0.0000,0.0000,0.0000000,0.0000000,-1.0000000,10.0000,0.0600,0.5000,25.0000,0.0000
GOTO/10.0000,0.0000,0.0000
$$ 3. TIMES,3 about -Z: 3 turns in all (2 full turns and 90 degrees), 5 mm down, to (0,10,-5).
CIRCLE/0.0000,0.0000,-5.0000,0.0000000,0.0000000,-1.0000000,10.0000,0.0600,0.5000,25.0000,0.0000,TIMES,3
GOTO/0.0000,10.0000,-5.0000
$$ The lead-out leaves along -X, the tangent of that arc at (0,10).
GOTO/-5.0000,10.0000,-5.0000
END-OF-PATH
