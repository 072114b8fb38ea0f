$$ An MSYS whose X and Y axes are parallel.
MSYS/0,0,0,1,0,0,1,0,0
GOTO/1,2,3
