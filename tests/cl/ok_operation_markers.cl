$$ The operation markers of several CAM systems; each starts an operation in place.
TOOL PATH/PLANAR_MILL,TOOL,MILL-10
$$ OPERATION NAME : Drilling.1
$$-> FEATNO / 32
PPRINT/BEGIN-SECTION,MACHINING
PPRINT/BEGIN-SECTION,TOOL
OPFEATSTART/Contour Mill1
GOTO/0,0,0
