"""Rigs and labelled cases that both the tests and the benches use: the server in a process of its own, a real
browser, an impaired network link, spoken commands, and the command sets with the plans they should give. The
benches (`bench/`) measure with them; the tests check with them and never import `bench`."""
