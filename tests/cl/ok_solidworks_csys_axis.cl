$$ SOLIDWORKS CAM set-ups: the third column of each CSYS (3x4, row by row) is the set-up's tool
$$ axis, which the 3-value GOTOs after it take (shimemcunha.apt: a tilted set-up, then one about
$$ +Z). A first set-up on the side face, its axis +X, then one from the top, drilling along +Z.
PARTNO/1
UNIT/MM
CUTTER/10.,0,5.,0,0,0,40.
LOAD/TOOL,1
SPINDL/3000,RPM,CLW
TRNTYP/WORLD,0,0,0
CSYS/0,0,1.,0,1.,0,0,0,0,1.,0,0
RAPID/
GOTO/120.,20.,-30.
FEDRAT/500.,MMPM
GOTO/100.,20.,-30.
GOTO/100.,40.,-30.
RAPID/
GOTO/120.,40.,-30.
TRNTYP/WORLD,0,0,0
CSYS/1.,0,0,0,0,1.,0,0,0,0,1.,0
RAPID/
GOTO/10.,10.,25.
CYCLE/INIT
CYCLE/DRILL,FEDTO,5.,MMPM,100.,RAPTO,3.,RTRCTO,25.,DWELL,0
GOTO/10.,10.,0
CYCLE/OFF
RAPID/
GOTO/10.,10.,25.
