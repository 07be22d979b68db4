"""mgdata.tasks"""
