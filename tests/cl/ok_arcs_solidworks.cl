PARTNO/1
UNIT/MM
$$ SOLIDWORKS CAM (TRNTYP, CSYS): 6-value CIRCLE, no radius; arcs run counter-clockwise about
$$ the axis vector written.
TRNTYP/WORLD,0,0,0
CSYS/1.,0,0,0,0,1.,0,0,0,0,1.,0
FEDRAT/1000.,MMPM
GOTO/10.,-5.,0
GOTO/10.,0,0
CIRCLE/0,0,0,0,0,1.
GOTO/0,10.,0
$$ Axis -Z: clockwise seen from +Z, back to (10,0,0).
CIRCLE/0,0,0,0,0,-1.
GOTO/10.,0,0
GOTO/10.,-5.,0
