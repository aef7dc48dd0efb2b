"""The metaheuristics of Stryczek's comparison (2014): CRIPSO, PSO, GA, COA and cuckoo search."""
