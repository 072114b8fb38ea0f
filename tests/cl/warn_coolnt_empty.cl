$$ COOLNT with a slash and no minor word (NX writes this).
COOLNT/
GOTO/1,2,3
