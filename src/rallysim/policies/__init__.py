"""Controllers that act in RallySim's envs: scripted, random and (later) trained policies."""

from rallysim.policies.scripted import ScriptedController

__all__ = ["ScriptedController"]
