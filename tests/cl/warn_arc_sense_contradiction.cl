$$ Siemens NX (TOOL PATH): arcs run clockwise about their axis; this one has a lead-out that
$$ leaves it counter-clockwise.
TOOL PATH/CONTOUR,TOOL,MILL-20
FEDRAT/MMPM,1000
GOTO/10,0,0
CIRCLE/0,0,0,0,0,1,10,0.06,0.5,25,0
GOTO/0,-10,0
GOTO/5,-10,0
END-OF-PATH
