"""Who may do what: users with hashed secrets, browser logins and API tokens, the viewer and operator roles, and
the one operator in control at a time."""
