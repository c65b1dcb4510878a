"""The iguana body: skeleton, markers, tetrahedral soft-body model, springs, skin weights."""
