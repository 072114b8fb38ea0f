$$ The feed value and its unit word come in either order.
FEDRAT/MMPM,250
GOTO/1,0,0
FEDRAT/250,MMPM
GOTO/2,0,0
FEDRAT/ 250.0000,MMPM
GOTO/3,0,0
