$$ A negative feed.
FEDRAT/-100,MMPM
GOTO/1,2,3
