$$ FROM sets the start point and tool axis; GODLTA moves by a vector, or along the tool axis.
$$ Before any tool change or move a FROM is where the tool starts, not a move; after one, a move.
FROM/0,0,100,0,0,1
FEDRAT/MMPM,300
GOTO/10,20,30
GODLTA/0,0,5
GODLTA/-5
GOTO/10,20,30,0,1,0
GODLTA/2
FROM/10,22,60
