"""Reading commands in everyday wording: tokens, the words people use (lexicon), steps in order (clauses), what
each step asks (intents) and which things in the world its names mean (names). The rules planner puts them
together."""
