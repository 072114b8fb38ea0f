$$ Text after a single $ is ignored (classic APT).
GOTO/1,2,$ contact point
3
