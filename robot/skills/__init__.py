"""What plan steps do (navigate, detect, pick, place, the simple actions), over the small protocols of
`robot.skills.body` only."""
