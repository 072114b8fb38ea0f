$$ A SOLIDWORKS CAM CSYS whose third column (the set-up's tool axis) is zero.
TRNTYP/WORLD,0,0,0
CSYS/1.,0,0,0,0,1.,0,0,0,0,0,0
GOTO/1,2,3
