$$ RAPID applies to the next motion only; the programmed feed then resumes.
FEDRAT/MMPM,500
GOTO/0,0,0
RAPID
GOTO/0,0,50
GOTO/10,0,50
GOTO/10,10,50
RAPID
GOTO/0,0,50
