"""One compiled step per player kind: the bodies' motion, the shuttle's flight, the face frame,
the swept test and the judging of N games, around MuJoCo's step of the one batched model."""
