$$ GOTO takes 3 values (x,y,z) or 6 (x,y,z,i,j,k), not 4.
GOTO/1,2,3,4
