$$ CATIA V5 breaks records at a fixed column, here inside the k of the tool axis (0.752602).
MULTAX
LOADTL/1
FROM  / -26.370000,  -1.310773,  50.000000,   0.000000,   0.000000,   1$
.000000
GOTO  /  -5.673572,  -1.310773,  13.476254,  -0.655944,   0.057682,   0$
.752602
PPRINT/(=====================================================$
=======)
