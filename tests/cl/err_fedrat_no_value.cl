$$ FEDRAT with a unit and no value.
FEDRAT/MMPM
GOTO/1,2,3
