$$ A trailing comma after the last coordinate.
GOTO/1,2,3,
