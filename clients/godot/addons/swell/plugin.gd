@tool
extends EditorPlugin
# Registers the addon's nodes in the editor's "Add Node" dialog. Everything else in the addon is
# plain scripts that work without the plugin enabled (preload them by path).


func _enter_tree() -> void:
	add_custom_type("SwellClient", "Node", preload("swell_client.gd"), null)
	add_custom_type("SwellSession", "Node", preload("swell_session.gd"), null)
	add_custom_type("SwellOcean", "Node3D", preload("swell_ocean.gd"), null)


func _exit_tree() -> void:
	remove_custom_type("SwellOcean")
	remove_custom_type("SwellSession")
	remove_custom_type("SwellClient")
