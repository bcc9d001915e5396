# Transfer function for T1 MRI brain renders (README, "Real data"): dark CSF
# and background transparent, grey and white matter opaque and warm.
domain 0 255
step 1
point 0 0 0 0 0
point 30 0 0 0 0
point 45 150 110 95 0.02
point 70 235 205 185 0.25
point 100 255 240 225 0.6
point 255 255 255 255 0.8
