"""Values and transforms: the formula language and the transform chain, pure maths."""
