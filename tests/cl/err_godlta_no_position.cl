$$ An incremental move before any GOTO or FROM.
GODLTA/0,0,5
GOTO/1,2,3
