"""The optimal control problem: scenario, collocation, initial loop and the NLP."""
