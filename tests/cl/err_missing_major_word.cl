$$ Arguments with no major word before the slash.
/1,2,3
